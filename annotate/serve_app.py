"""The script ``annotate serve`` hands to ``streamlit run``: three lines that call
:func:`annotate.app.main`.

Streamlit compiles its script again for every new session and executes it on every full
rerun; the rater app itself is a module, imported once per server process, so neither its
compilation nor the definition of its pages, fragments and caches is repeated per rater.
"""

from annotate.app import main

if __name__ == "__main__":  # streamlit runs the script as __main__; imports do nothing
    main()
