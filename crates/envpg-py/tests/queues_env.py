"""A Python port of `examples/queues` (the Rust `queues` environment), float operation for float
operation and draw for draw, so that training on it gives the Rust environment's result bit for
bit. Also the test suite's environment written in Python."""

import envpg


class Queues(envpg.Env):
    """Two servers whose speeds ζ are designed, jobs routed between them (discounted)."""

    n_actions = 3
    zeta_names = ["speed1", "speed2"]
    zeta_low = [0.05, 0.05]
    zeta_high = [0.95, 0.95]

    def __init__(self, buffer=4, lam=0.6, hold=1.0, w1=2.0, w2=2.5, reject=8.0, gamma=0.95, model=True):
        self.buffer, self.lam, self.hold, self.w, self.reject, self.gamma = buffer, lam, hold, (w1, w2), reject, gamma
        self.n_states = (buffer + 1) * (buffer + 1)
        self.cost_scale = hold * buffer / (1.0 - gamma)
        if not model:
            # A black box: without these the oracle and exact evaluation refuse it.
            self.outcomes = None
            self.initial_distribution = None

    def lengths(self, s):
        return [s // (self.buffer + 1), s % (self.buffer + 1)]

    def state(self, q):
        return q[0] * (self.buffer + 1) + q[1]

    def valid_actions(self, s):
        q = self.lengths(s)
        return [a for a in range(3) if a == 2 or q[a] < self.buffer]

    def is_terminal(self, s):
        return False

    def initial_state(self, rng):
        return 0

    def exploring_start(self, rng):
        return rng.integers(0, self.n_states)

    def cost(self, s, a, zeta):
        q1, q2 = self.lengths(s)
        speed = self.w[0] * zeta[0] * zeta[0] + self.w[1] * zeta[1] * zeta[1]
        return self.hold * float(q1 + q2) + speed + (self.reject * self.lam if a == 2 else 0.0)

    def next(self, s, a, arrive, d):
        q = self.lengths(s)
        for j in range(2):
            q[j] -= 1 if (d[j] and q[j] > 0) else 0
        if arrive and a < 2:
            q[a] += 1
        return self.state(q)

    def step(self, s, a, zeta, rng):
        arrive = rng.random() < self.lam
        d = [rng.random() < zeta[0], rng.random() < zeta[1]]
        return self.next(s, a, arrive, d), self.cost(s, a, zeta)

    def initial_distribution(self):
        return [(0, 1.0)]

    def outcomes(self, s, a, zeta, grad):
        cost = self.cost(s, a, zeta)
        busy = [q > 0 for q in self.lengths(s)]
        nxt, prob, dprob = [], [], []

        def f(on, b, z):
            return 1.0 if not b else (z if on else 1.0 - z)

        def df(on, b):
            return 0.0 if not b else (1.0 if on else -1.0)

        for arrive in (False, True):
            for d1 in (False, True):
                for d2 in (False, True):
                    if (d1 and not busy[0]) or (d2 and not busy[1]):
                        continue
                    pa = self.lam if arrive else 1.0 - self.lam
                    f1, f2 = f(d1, busy[0], zeta[0]), f(d2, busy[1], zeta[1])
                    t = self.next(s, a, arrive, [d1, d2])
                    if t in nxt:
                        k = nxt.index(t)
                    else:
                        nxt.append(t)
                        prob.append(0.0)
                        dprob.append([0.0, 0.0])
                        k = len(nxt) - 1
                    prob[k] += pa * f1 * f2
                    dprob[k][0] += pa * df(d1, busy[0]) * f2
                    dprob[k][1] += pa * f1 * df(d2, busy[1])
        costs = [cost] * len(nxt)
        if not grad:
            return nxt, prob, costs
        dcost = [[2.0 * self.w[0] * zeta[0], 2.0 * self.w[1] * zeta[1]] for _ in nxt]
        return nxt, prob, costs, dprob, dcost


class ClusteredQueues(Queues):
    """Queues with a clustered design hook: service rates drawn near the middle of their range."""

    def __init__(self, buffer=2, outside=False):
        super().__init__(buffer=buffer)
        self.outside = outside

    def clustered_design(self, rng):
        if self.outside:
            return [2.0, 0.5]
        return [0.4 + 0.2 * rng.random(), 0.4 + 0.2 * rng.random()]
