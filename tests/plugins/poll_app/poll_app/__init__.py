"""A live poll on the wall: a bar and a code per choice, one vote per phone."""
