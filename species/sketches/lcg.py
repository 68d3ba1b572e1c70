"""A reproducible random stream for the sketch scripts (the same numbers on every Python)."""


class Lcg:
    """Numerical Recipes LCG: reproducible on every Python."""

    def __init__(self, seed):
        self.state = seed & 0xFFFFFFFF

    def uniform(self, a=0.0, b=1.0):
        self.state = (1664525 * self.state + 1013904223) & 0xFFFFFFFF
        return a + (b - a) * self.state / 2.0**32
