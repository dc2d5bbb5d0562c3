"""Design checks of the lining: section capacity (``capacity``) and the closed-form seismic ovaling
methods (``ovaling``). Pure Python, SI units; docs/user_guide.md "Lining design checks" describes both."""
