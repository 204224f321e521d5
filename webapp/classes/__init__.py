"""Classes held at a wall: Start class to End class, and the roll of who joined."""
