"""The settings.

Owns the settings dataclasses and their validation (``settings``), the TOML file (``file``: where it
lives, line-exact read errors, atomic writes, stale temporary files), and the live store (``store``:
validated, saved, then published to the running server).

May import ``zwo.firmware`` (presets) and ``_exceptions`` only.
"""
