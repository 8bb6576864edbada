"""Configuration: the schema (frozen dataclasses), loading from YAML/JSON, validation, hashing."""

from moonbot.config.load import ConfigError, config_hash, default_config_path, load_config, parse_overrides, parse_yaml
from moonbot.config.schema import Config

__all__ = [
    "Config",
    "ConfigError",
    "config_hash",
    "default_config_path",
    "load_config",
    "parse_overrides",
    "parse_yaml",
]
