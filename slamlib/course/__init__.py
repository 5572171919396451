"""The course's own machinery (exercise checkers, chapter helpers); the library never imports it."""
