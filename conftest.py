"""Repository-level pytest configuration: which files are not test modules."""

# annotate/app.py is a Streamlit script (it runs on import); benchmarks are run by hand.
collect_ignore = ["annotate/app.py", "benchmarks", "build", "docs"]
