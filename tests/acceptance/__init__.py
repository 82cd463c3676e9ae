"""Known-truth acceptance engine: seeded problems whose true parameters are known
(`acceptance.generator`), run through ``vibupdate run`` and ``vibupdate.update`` and judged as
a user judges them (`acceptance.runner`)."""
