"""Reference controllers, all batched, behind one interface (DESIGN.md principle 2).

The geometric controller, geometric + NDOB, cascaded PID and sliding-mode control land here
with the controllers issue; until then ``quad-dob demo`` flies open-loop hover thrust.
"""
