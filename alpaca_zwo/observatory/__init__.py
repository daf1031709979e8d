"""The observatory around the mount: the Alpaca SafetyMonitor (and roof) the mount obeys (issue 35).

``watch.SafetyWatch`` polls the configured SafetyMonitor's IsSafe and the roof's (an Alpaca Dome's)
ShutterStatus, turns the answers, their age and the errors into one verdict and writes it into the
interlock gate every motion start asks (``motion/interlock.py``). ``response.SafetyResponder`` carries out
``[safety] on_unsafe`` when the verdict turns unsafe: stop everything, then park with tracking off, or
stop with tracking off, on every telescope, connecting a mount nobody holds and waiting for one whose
link is down. Finding the devices on the LAN (the page's button) is ``alpaca/finder.py``.

May import telescope, motion, config, alpaca, clients (a floor above the telescope, beside the bridges).
"""

from .response import SafetyResponder
from .watch import SafetyWatch

__all__ = ["SafetyResponder", "SafetyWatch"]
