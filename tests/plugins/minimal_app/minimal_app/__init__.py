"""The smallest tagwall app: a sun across the wall and one code beside it."""
