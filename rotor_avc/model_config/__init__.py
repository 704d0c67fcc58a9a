"""Each model's config sections read and validated into the numbers its builder in
:mod:`rotor_avc.models` takes (one module per ``model:`` name, with the top-level keys it reads,
``MODEL_KEYS``, and what the machine built from it supports, ``SUPPORTS``)."""
