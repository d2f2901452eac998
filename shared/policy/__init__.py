"""The policy network and its checkpoints, shared by the trainer and the rollout/evaluation workers.

`racer.shared.policy.networks`: DeepRacer's actor-critic (`build_actor_critic`, `ActorCritic.act`).
`racer.shared.policy.checkpoints`: the `model/` key layout in a store (`CheckpointStore`).
"""
