"""Campaigns of simulated runs on Dask (tribo-campaign; docs/campaigns.md)."""

from .spec import Campaign, RunTask, SpecError, load_spec, set_field

__all__ = ["Campaign", "RunTask", "SpecError", "load_spec", "set_field"]
