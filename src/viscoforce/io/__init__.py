"""Reading files into SI arrays (conversions happen here, at the boundary)."""
