"""An app that reaches outside its own name, which tagwall refuses to load."""
