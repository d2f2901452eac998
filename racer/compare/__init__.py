"""`racer compare`: training runs side by side on one self-contained page."""
