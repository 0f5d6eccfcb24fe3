"""The simulator's node: its robots' topics and frames, injected faults, and lockstep stepping."""
