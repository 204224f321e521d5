"""The brain atlas: the MNI brain across the wall with a red pin on each region, a quiz
whose answers only instructors see early, and a tutor per user group.

The wall state says what is shown: ``volume`` and ``view`` (one of the presets in
``content/brain_atlas/views.yaml``, or wherever the instructor turned it), ``mode``
(quiz or tutor), ``tag_set`` (the K-5 pins or the full set) and, in the brain's slot
(``state``), ``quiz_round``.
Pins are computed from the label volume for exactly that picture (``pins``), so a pin
always marks a point of its region the wall shows. Pins carry numbers, never names:
a pin's code, label and parameters tell nothing about the answer, and each quiz round
numbers the pins in a fresh random order under fresh codes (``quiz``).
"""
