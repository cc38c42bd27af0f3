"""Develop: give every panel a developable surface (a k x k sample grid) and measure it."""
