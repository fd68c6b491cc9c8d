"""analysis stage of the NVRQ toolkit."""
