"""bsrflow: granular flows with the BSR integro-PDE model."""
__version__ = "0.1.0"
