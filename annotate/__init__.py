"""annotate stage of the NVRQ toolkit."""
