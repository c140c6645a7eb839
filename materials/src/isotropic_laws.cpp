// isotropic_laws: being written
