"""The policy network and its checkpoints, shared by the trainer and the rollout/evaluation workers.

`racer.shared.policy.networks`: DeepRacer's clipped-PPO actor-critic (`build_actor_critic`, `ActorCritic.act`).
`racer.shared.policy.sac_networks`: DeepRacer's SAC policy, twin Q and V networks on the same embedders.
`racer.shared.policy.factory`: `build_network(config)`, the one place that picks between them.
`racer.shared.policy.checkpoints`: a run's checkpoints in a store (`CheckpointStore`: save, load, pointer, retention);
`manifest`, `optimizer_files`, `onnx_export` and `best_and_last` are its parts, one job each. The keys themselves
are `racer.shared.model_layout`'s.
"""
