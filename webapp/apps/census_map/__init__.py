"""The census map: census tracts across the whole wall, a code on every tract big
enough to carry one, group toggles on the menu screen, description balloons, pages
sized to each visitor's information class, and KML so Google Earth stays a client.

The data set is in the database (``store``), its geometry on a flat plane
(``mapview``); the wall state says which data set is shown (``dataset``), the view
(pan and zoom), which groups are hidden (``layers``) and which balloons are open.
"""
