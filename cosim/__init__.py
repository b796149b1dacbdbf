"""Systems of FMUs: SSP and OSP system files, and masters that run them (fmpy, libcosim)."""
