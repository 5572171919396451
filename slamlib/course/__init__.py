"""The course's own machinery (chapter studies, exercise checkers); it imports the library,
the library never imports it."""
