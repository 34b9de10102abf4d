"""Ray RLlib: scale-out training (:mod:`.backend`), its connectors (:mod:`.connectors`) and the
agent of a checkpoint (:mod:`.agent`). ray is imported only here, and only when used."""
