"""Physics: surface-force laws, materials and geometry."""
