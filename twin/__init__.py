"""TacTip digital twin."""
