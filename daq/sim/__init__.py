"""The simulated rig behind `sim://`: carts on springs, a scripted hand, an encoder box.

Modules: `options` (the URL options, `describe_options()`), `physics` (the chain and its
integrator), `hand` (the scripted cases), `rig` (device, dialects, faults). The pyserial
handler is `daq.serial_handlers.protocol_sim`. numpy only.
"""

from daq.sim.options import SimOptionError, SimOptions, describe_options, parse_sim_url
from daq.sim.rig import Rig, RigStats

__all__ = ["Rig", "RigStats", "SimOptionError", "SimOptions", "describe_options", "parse_sim_url"]
