"""tagwall as an LTI 1.3 Advantage tool: launches from a course start and join a wall's
class, the course's roster fills it, and its scores go back to the gradebook
(docs/campus.md)."""
