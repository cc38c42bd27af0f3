"""Develop: give every panel a developable surface (a k x k sample grid) and measure it.

Methods: ``project`` samples each panel on the design surface (exact for surfaces that are
already developable, such as a barrel vault) and measures how developable the result is.
"""

from .project import develop

__all__ = ["develop"]
