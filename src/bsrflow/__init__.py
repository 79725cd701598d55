"""bsrflow: granular flows with the BSR (Blackmore-Samulyak-Rosato) integro-PDE model.

Physics (``bsrflow.physics``: kernels, applied motions, the model, scenarios, DEM), numerics
(``bsrflow.numerics``: grids, quadrature, steppers, the compiled loop) and tools
(``bsrflow.analysis``, ``bsrflow.io``, ``bsrflow.cli``) are kept apart.  Every quantity is
in SI units.
"""

__version__ = "0.1.0"

from ._numba_cache import use_versioned_cache_dir  # noqa: E402

NUMBA_CACHE_DIR = use_versioned_cache_dir()
"""The folder of this version's compiled functions (:mod:`bsrflow._numba_cache`), or None when
numba's default (or the user's ``NUMBA_CACHE_DIR``) is used."""

from ._numba_threads import prefer_leak_free_layers, prefer_passive_omp_wait  # noqa: E402

NUMBA_THREADING_LAYER_PRIORITY = prefer_leak_free_layers()
"""numba's threading layers in the order the package prefers them (:mod:`bsrflow._numba_threads`:
tbb leaked memory at every parallel launch here), or None when the user's environment chose."""
OMP_WAIT_POLICY = prefer_passive_omp_wait()
"""``PASSIVE``, set for GNU OpenMP (its threads spinning between parallel regions slowed a shared
machine's runs, :mod:`bsrflow._numba_threads`), or None when the user's environment set it."""

from .numerics.grid import Grid1D  # noqa: E402
from .numerics.grid_nd import GridND  # noqa: E402
from .numerics.solver import Scheme, Simulation, SimulationError, SimulationResult  # noqa: E402
from .numerics.solver_nd import ResultND, SimulationND  # noqa: E402
from .physics.kernels import Kernel, walton_braun, walton_braun_from_contact, zero_kernel  # noqa: E402
from .physics.kernels_nd import BSRModelND, KernelND, walton_braun_nd  # noqa: E402
from .physics.model import BSRModel  # noqa: E402
from .physics.motion import AppliedMotion, HalfSineTaps, Rest, SinusoidalVibration  # noqa: E402

__all__ = [
    "Grid1D", "Scheme", "Simulation", "SimulationError", "SimulationResult", "Kernel", "walton_braun",
    "walton_braun_from_contact", "zero_kernel", "BSRModel", "AppliedMotion", "HalfSineTaps", "Rest",
    "SinusoidalVibration", "GridND", "SimulationND", "ResultND", "BSRModelND", "KernelND", "walton_braun_nd",
    "__version__",
]
