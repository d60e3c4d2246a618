"""Co-simulation, float reference, model audit and bench tool for Bowden-cable tension control."""

__version__ = "0.1.0"
