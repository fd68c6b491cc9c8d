"""Names that `vulture --min-confidence 80` reports as unused but that are used, each with why.

vulture reads this file with the packages (pyproject.toml's [tool.vulture]); a name written
here counts as used. Keep it under 30 entries, and give every entry its reason.
"""

# annotate/app.py, close_uploads: the stand-in for Streamlit's UploadedFileManager.add_file
# keeps its signature, and Streamlit passes session_id by keyword.
session_id  # noqa: B018, F821
