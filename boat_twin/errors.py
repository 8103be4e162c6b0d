"""The one exception type for bad user input: the CLI turns it into one line and exit code 2."""


class InputError(Exception):
    """Bad input from the user (a file, a field, a flag); the message names it and says what is wrong."""
