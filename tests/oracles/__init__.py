"""Reference implementations the tests check the package against (not shipped in armlab)."""
