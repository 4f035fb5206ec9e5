"""Finite-element rotors: the ``[shaft]`` schema (``schema``), the symbolic Timoshenko and
disk element matrices (``elements``), their assembly with linear bearings (``assembly``) and
the reader of ROSS rotor files (``ross_import``)."""
