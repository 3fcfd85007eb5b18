"""The training config: YAML files read into frozen dataclasses, checked on load.

| module | what |
|---|---|
| ``files`` | finding, reading and writing config files; every config name is importable from here |
| ``schema`` | the config's sections as frozen dataclasses, each checking its YAML |
| ``agent`` | the ``agent`` section: what the policy sees and sends beside the env's own |
| ``checks`` | ``ConfigError`` and the typed readers of YAML values |

Nothing is imported here: ``files`` and ``schema`` import the learners' algorithm table, which
imports ``checks``.
"""
