"""Browser viewer: what the lab shows in RViz, served on http://127.0.0.1:8765 by the `viewer` node."""
