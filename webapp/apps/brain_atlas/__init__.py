"""The brain atlas: the MNI brain across the wall with a pin on each region, a quiz
whose answers only instructors see early, and a tutor per user group.

Built so far: its content (``content``) and tolerant answer matching (``matching``).
"""
