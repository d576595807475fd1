"""Real-rig backend."""
