"""One physics of the lab's carts, shared by the simulated rig (`daq.sim`), the simple
identification, PEM's physical start and the diagnosis.

Modules: `lti` (hand-derived linear models, transfer functions, modes), `steppers` (RK4 and
explicit Euler, the handout's Euler with Coulomb friction), `chain` (mass-normalised chain
matrices, exact linear free response), `free` + `kernel` (the free response with dry,
pre-sliding, viscous and quadratic friction, cubic springs and inputs, batched, compiled),
`rig` (the sim rig's stepper with hand-held carts), `measures` (fit %, noise, spectral
peaks). Pure numerics: no clocks, files or transports.
"""

from __future__ import annotations

from ident.physics.free import NonlinearTerms, simulate_free
from ident.physics.lti import (
    InputStructure,
    Mode,
    SingleCart,
    StateSpace,
    TwoCartChain,
    describe,
    modes_of,
    transfer_functions,
)
from ident.physics.measures import fit_percent, noise_std, spectral_peaks, spectrum
from ident.physics.steppers import (
    Method,
    euler,
    euler_coulomb,
    linear_step_map,
    linear_step_response,
    rk4,
)

__all__ = ["InputStructure", "Method", "Mode", "NonlinearTerms", "SingleCart", "StateSpace", "TwoCartChain",
           "describe", "euler", "euler_coulomb", "fit_percent", "linear_step_map", "linear_step_response",
           "modes_of", "noise_std", "rk4", "simulate_free", "spectral_peaks", "spectrum", "transfer_functions"]
