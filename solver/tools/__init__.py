"""The user's entry points over the run: the command line (``cli``), the Python
API (``api``), parameter sweeps (``sweep``) and plots (``plot``).
"""
