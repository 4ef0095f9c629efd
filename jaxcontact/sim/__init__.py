"""A rigid tool ploughing an elastic workpiece: jaxcontact inside a JAX simulation.

Also ``jaxcontact.sim.hertz``: a rigid cylinder pressed into an elastic
block, solved to equilibrium by Newton's method and set against Hertz.
Apart from the detection library: it uses only jaxcontact's public names.
"""

from jaxcontact.sim import hertz as hertz
from jaxcontact.sim.elastic import Material as Material
from jaxcontact.sim.elastic import Mesh as Mesh
from jaxcontact.sim.elastic import workpiece_mesh as workpiece_mesh
from jaxcontact.sim.ploughing import MASS_SCALED_STEEL as MASS_SCALED_STEEL
from jaxcontact.sim.ploughing import Controls as Controls
from jaxcontact.sim.ploughing import Final as Final
from jaxcontact.sim.ploughing import History as History
from jaxcontact.sim.ploughing import Ploughing as Ploughing
from jaxcontact.sim.ploughing import mean_cutting_force as mean_cutting_force
from jaxcontact.sim.ploughing import ploughing as ploughing
from jaxcontact.sim.ploughing import run as run
from jaxcontact.sim.ploughing import simulate as simulate
from jaxcontact.sim.tool import tool_outline as tool_outline
from jaxcontact.sim.tool import tool_surface as tool_surface
