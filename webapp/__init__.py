"""tagwall web application: app factory, settings, wall state, routes."""
