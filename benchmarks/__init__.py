"""Load and serial-budget benchmarks for alpaca-zwo (not part of the pass/fail test suite).

``python -m benchmarks.run --quick`` is the smoke check; ``python -m benchmarks.run`` the full run.
Results go to ``benchmarks/results/`` as JSON plus a rendered Markdown table; see BENCHMARKS.md.
"""
