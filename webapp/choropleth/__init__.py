"""Choropleth maps: areas coloured by a value cut into classes (``classes``), in
ColorBrewer's colour-blind-safe schemes (``palettes``). Nothing here knows the census:
the wall state names a :class:`~webapp.choropleth.classes.Theme`, the census map applies it.
"""
