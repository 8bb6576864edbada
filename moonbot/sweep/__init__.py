"""The sweep: which scenes and tasks a config asks for, in a fixed order, each with the config
it renders with and a seed taken from its identity alone (never from the worker that runs it)."""

from moonbot.sweep.tasks import Task, scene_seed, task_config, tasks

__all__ = ["Task", "scene_seed", "task_config", "tasks"]
