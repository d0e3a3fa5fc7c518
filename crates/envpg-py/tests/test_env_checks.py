"""`envpg.check_env`: a Python model's derivatives against central differences and its sampler
against its probabilities — the test environment passes, broken ones are named."""

import pytest
from broken_envs import WrongDerivative, WrongSampler
from queues_env import Queues

import envpg


def test_the_python_queues_model_passes_every_check():
    for zeta in ([0.3, 0.7], [0.9, 0.1]):
        envpg.check_env(Queues(), zeta, states=[0, 6, 24], samples=20_000)
    envpg.check_env("flpo-n10m4")


def test_a_wrong_derivative_is_named():
    with pytest.raises(envpg.EnvCheckError, match="ζ1"):
        envpg.check_env(WrongDerivative(), [0.3, 0.7])


def test_a_sampler_that_disagrees_with_its_model_is_named():
    envpg.check_env(WrongSampler(), [0.3, 0.7])  # the model alone is consistent
    with pytest.raises(envpg.EnvCheckError):
        envpg.check_env(WrongSampler(), [0.3, 0.7], states=[6], samples=20_000)


def test_checks_need_a_model_and_a_design_inside_the_bounds():
    with pytest.raises(envpg.InputError, match="no model"):
        envpg.check_env(Queues(model=False))
    with pytest.raises(envpg.InputError):
        envpg.check_env(Queues(), [2.0, 0.5])
