"""Wall geometry and the kiosk launcher for render nodes."""
