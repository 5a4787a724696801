"""Runnable studies of the EEA (``python -m eea.scripts.<name>``); not imported by ``eea``."""
