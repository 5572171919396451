"""The course's own machinery (chapter studies, their stored evidence, chapter plots).

It imports the library; the library never imports it.

- ``evidence``  the 100-seed studies behind the consistency lessons of chapters 02, 03, 05
  and 07, stored as JSON in ``data/evidence`` by ``tools/make_evidence.py``
"""
