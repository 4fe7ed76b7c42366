"""Training, evaluation, the paper reproduction and the ``quad-dob`` command line."""
