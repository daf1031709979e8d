"""The mount's language and its line.

Owns the ZWO command table and error codes (``protocol``), the values on the wire and their text
forms (``wire_values``), the request framer that cuts a byte stream into commands as the mount does
(``request_framer``), the byte pipe with its arbiter and urgent lane (``link``), firmware presets
and feature gates (``firmware``), finding a mount on this machine's ports (``devices``), and the
owner's read-only survey of a mount (``survey``). Shared by the driver, the bridges and the emulator.

May import only ``alpaca_zwo._exceptions``: nothing here knows Alpaca, motion or the configuration.
"""
