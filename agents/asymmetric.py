"""The class path an SB3 model of a privileged-critic run names: a model zip pickles its policy
class by module and name, and runs saved before the policy moved to
:mod:`cepam_gym_agents.learners.asymmetric` name this module (``agent.privileged_critic``, the
shipped ``quick`` config). Kept so that those runs still load; new code imports the policy from
:mod:`cepam_gym_agents.learners.asymmetric`."""

from .learners.asymmetric import ActorColumns, AsymmetricActorCriticPolicy

__all__ = ["ActorColumns", "AsymmetricActorCriticPolicy"]
