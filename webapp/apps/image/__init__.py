"""The image app: an instructor's image, from a phone photo to a 30,000 px scan, across
the wall as a tile pyramid each display fetches its own share of (docs/image.md)."""
