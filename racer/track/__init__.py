"""`racer track ...`: list, inspect and plot tracks."""
