"""A tiny tagwall app: a greeting across the wall and one code that opens it on a phone."""
