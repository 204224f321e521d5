"""The engine: the wall state, its one door for changes, the hub that commits and
publishes them in order, the event bus and the websocket protocol."""
