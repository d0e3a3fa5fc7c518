"""Environments that fail in the ways the tests check."""

from queues_env import Queues


class Raises(Queues):
    """`step` raises after a number of steps (in every worker)."""

    def __init__(self, after=50):
        super().__init__()
        self.after, self.count = after, 0

    def step(self, s, a, zeta, rng):
        self.count += 1
        if self.count > self.after:
            raise ZeroDivisionError("the simulator broke")
        return super().step(s, a, zeta, rng)


class ReturnsNaN(Queues):
    def step(self, s, a, zeta, rng):
        return 0, float("nan")


class LeavesTheStates(Queues):
    def step(self, s, a, zeta, rng):
        return self.n_states + 3, 1.0


class BadConstructor(Queues):
    """Builds here, but not from its recorded arguments (as in a process without the file)."""

    def __init__(self, simulator=None):
        super().__init__()
        if simulator is not None:
            open(simulator)

    def config(self):
        return {"simulator": "/no/such/simulator-file"}


class HugeStates(Queues):
    """Claims more states than episodes can name."""

    def __init__(self):
        super().__init__()
        self.n_states = 2**40


class BadActions(Queues):
    def valid_actions(self, s):
        return [2, 0]


class Slow(Queues):
    """Sleeps in every step: a run long enough to interrupt."""

    def step(self, s, a, zeta, rng):
        import time

        time.sleep(0.0001)
        return super().step(s, a, zeta, rng)


class WrongDerivative(Queues):
    """`outcomes` reports ∂c/∂ζ₂ twice too large."""

    def outcomes(self, s, a, zeta, grad):
        out = super().outcomes(s, a, zeta, grad)
        if grad:
            for row in out[4]:
                row[1] *= 2.0
        return out


class WrongSampler(Queues):
    """`step` draws arrivals at a different rate than `outcomes` says."""

    def step(self, s, a, zeta, rng):
        arrive = rng.random() < 0.9
        d = [rng.random() < zeta[0], rng.random() < zeta[1]]
        return self.next(s, a, arrive, d), self.cost(s, a, zeta)


class TakesStar(Queues):
    """Built from positional `*args`, which a run's processes cannot be given again."""

    def __init__(self, *sizes):
        super().__init__()
