"""The torus as the invariant circle of the shaft-period map: quasi-periodic shooting
(``solve``: ``ShaftMap``, ``solve_circle``, ``circle_dataset``) and the circle branch family
of the continuation engine (``continuation``). It lives in ``analysis.frequency``, not
beside periodic shooting in ``analysis.stability``, because it is a second method for the
same torus: it writes the torus Dataset and checks itself against the 2-D HB torus
(``torus``), which the stability layer may not import. Public names are importable from
``analysis.frequency``."""
