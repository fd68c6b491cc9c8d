"""The script ``annotate serve`` hands to ``streamlit run``: it closes the file-upload store
and calls :func:`annotate.app.main`.

Streamlit compiles its script again for every new session and executes it on every full
rerun; the rater app itself is a module, imported once per server process, so neither its
compilation nor the definition of its pages, fragments and caches is repeated per rater.

The rater app has no file uploader, yet Streamlit's ``/_stcore/upload_file/...`` route takes
files from any websocket session (measured: 5 x 100 MB took a server from 223 to 725 MB).
``annotate serve`` sets ``server.maxUploadSize`` to 0, which refuses every upload that says
its size (413); :func:`annotate.app.refuse_uploads` also makes the server's upload store
keep nothing, for a request that hides its size (an empty file with a long name, chunked).
"""

from annotate.app import main, refuse_uploads

if __name__ == "__main__":  # streamlit runs the script as __main__; imports do nothing
    refuse_uploads()
    main()
