"""``python -m alpaca_zwo.emulator``: the same as the ``alpaca-zwo-emulator`` console script."""

from __future__ import annotations

from .cli import main

raise SystemExit(main())
