#!/usr/bin/env bash
# Issue 26 step 1 (mechanical): move files, make packages, rewrite imports. Run from the repo root.
set -euo pipefail
mkdir -p alpaca_zwo/zwo alpaca_zwo/mount alpaca_zwo/telescope alpaca_zwo/config
# A module and a package of one name cannot coexist: move mount.py/telescope.py/config.py aside first.
git mv alpaca_zwo/mount.py alpaca_zwo/mount/operations.py
git mv alpaca_zwo/telescope.py alpaca_zwo/telescope/device.py
git mv alpaca_zwo/config.py alpaca_zwo/config/settings.py
for f in protocol wire_values request_framer link firmware devices; do git mv alpaca_zwo/$f.py alpaca_zwo/zwo/$f.py; done
git mv alpaca_zwo/mount_state.py alpaca_zwo/mount/state.py
git mv alpaca_zwo/estimator.py alpaca_zwo/mount/estimator.py
git mv alpaca_zwo/settings_cache.py alpaca_zwo/mount/settings_cache.py
git mv alpaca_zwo/telescope_connection.py alpaca_zwo/telescope/connection.py
git mv alpaca_zwo/telescope_caps.py alpaca_zwo/telescope/capabilities.py
git mv alpaca_zwo/actions.py alpaca_zwo/telescope/actions.py
git mv alpaca_zwo/config_file.py alpaca_zwo/config/file.py
git mv alpaca_zwo/store.py alpaca_zwo/config/store.py
git mv alpaca_zwo/listen_check.py alpaca_zwo/alpaca/listen_check.py
git mv alpaca_zwo/local_addresses.py alpaca_zwo/alpaca/local_addresses.py
for p in zwo mount telescope config; do printf '"""%s (docstring: see the plan)."""\n' "$p" > alpaca_zwo/$p/__init__.py; git add alpaca_zwo/$p/__init__.py; done
python3 "${REWRITE:-docs/plans/issue26-tools/rewrite.py}" .
