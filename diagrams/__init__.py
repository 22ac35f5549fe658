"""rpod.diagrams: the Scenario, the builders that wire it into Drake Diagrams, and simulate().

Importing the package registers the built-in controller plug-ins (rpod.diagrams.controllers)
and those other packages declare (entry point group `rpod.controllers`), so that a scenario's
`controller: !Tag {...}` can name any of them.
"""

from rpod.diagrams import controllers  # noqa: F401  (registration of the built-ins)
from rpod.diagrams.controller_seam import load_entry_points

load_entry_points()
