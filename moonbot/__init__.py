"""moonbot: physically grounded synthetic BOP datasets of regolith bags on the Moon.

Importing the package has no side effects; the compiled core is ``moonbot._core``.
"""

__version__ = "0.1.0"
