"""An example of a user's controller package for quad_dob_env (``docs/controllers.md``)."""
