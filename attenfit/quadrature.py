"""An independent check of the exact irradiance: the radiometric integral over the emitter's
visible surface by Gauss-Legendre quadrature. Implemented in `attenfit._truth._quadrature`.
"""

from ._truth._quadrature import irradiance as irradiance

__all__ = [
    "irradiance",
]
