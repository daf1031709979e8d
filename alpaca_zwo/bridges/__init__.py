"""Bridges: other programs' protocols served on top of the same Telescope as Alpaca.

Each bridge drives the mount only through the Telescope's public methods, so the limits,
parking rules, aborts and client reference counting that apply to Alpaca apply to it too.
"""
