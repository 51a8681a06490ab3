"""linsense.sim: the closed-loop drive simulator (plant, inverter and sensors in C around the
firmware controller).

``simulate(scenario) -> Result`` and ``simulate_many(scenarios, workers=N)``;
``simulate_to(out, scenario, trace=...)`` writes what ``linsense simulate`` writes; scenario files are
described in docs/simulator.md. The low-level C access is :mod:`linsense.sim.core`.
"""

from linsense.scenario.load import Scenario, load_scenario, scenario_from_dict
from linsense.sim.result import Result
from linsense.sim.simulation import simulate, simulate_many
from linsense.sim.to_folder import SimulateOutput, simulate_to

__all__ = ["Result", "Scenario", "SimulateOutput", "load_scenario", "scenario_from_dict", "simulate",
           "simulate_many", "simulate_to"]
