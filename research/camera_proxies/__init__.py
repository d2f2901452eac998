"""How close do racer's camera frames look to DeepRacer's, and does that predict transfer? (README.md)"""
