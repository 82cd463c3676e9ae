"""Known-truth acceptance engine: seeded problems whose true parameters are known
(`acceptance.generator`, `acceptance.families`), run through ``vibupdate run`` and
``vibupdate.update`` (`acceptance.runner`) and judged from what the engine computes itself
(`acceptance.judge`, `acceptance.determinacy`) against each family's criteria
(`acceptance.criteria`)."""
