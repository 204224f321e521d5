"""One quiz engine for every app that asks questions about what the wall shows."""
