"""`racer reward test`: a reward function checked over a whole track."""
