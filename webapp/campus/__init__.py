"""Campus identity beside tagwall's own accounts: staff through the institution's OpenID
providers (:mod:`webapp.campus.oidc`)."""
