"""The WGS84 ellipsoid, which Google Earth and CesiumJS draw: one home for the Earth
documents' views (``earth``) and the globe's camera (``globe``)."""

from __future__ import annotations

WGS84_A = 6_378_137.0  # its equatorial radius (m)
WGS84_F = 1 / 298.257223563  # its flattening
WGS84_E2 = WGS84_F * (2 - WGS84_F)  # its first eccentricity, squared
