"""Small problems with closed-form solutions, shared by the transcription tests."""

import casadi as ca

from ocpkit import Control, OptimalControlProblem, State


def min_energy_double_integrator() -> OptimalControlProblem:
    """min int_0^1 u^2 dt, x1' = x2, x2' = u, (0, 0) -> (1, 0): u = 6 - 12 t, x2 = 6t - 6t^2, J = 12."""
    return OptimalControlProblem(
        "min_energy",
        [State("x1", initial=0.0, final=1.0), State("x2", initial=0.0, final=0.0)],
        [Control("u")],
        lambda x, u, t: ca.vertcat(x[1], u[0]),
        tf=1.0,
        lagrange=lambda x, u, t: u[0] ** 2,
    )


def fixed_gain_leg(t0, tf, initial=(None, None), final=(None, None), parameters=None) -> OptimalControlProblem:
    """One leg of x'' = g u on [t0, tf] with running cost u^2 / 2, the gain g the product of the fixed
    ``parameters`` (default ``{"k": 1.0}``): two legs (0, 0) -> (1, 0) over [0, 1] with one gain cost J = 6 / g^2."""
    parameters = {"k": 1.0} if parameters is None else dict(parameters)
    names = list(parameters)

    def dynamics(x, u, t, p):
        gain = 1.0
        for name in names:
            gain = gain * p[name]
        return [x["v"], gain * u["u"]]

    return OptimalControlProblem(
        f"gain_{t0}",
        [State("x", initial=initial[0], final=final[0]), State("v", initial=initial[1], final=final[1])],
        [Control("u")],
        dynamics,
        t0=t0,
        tf=tf,
        lagrange=lambda x, u, t: u["u"] ** 2 / 2,
        parameters=parameters,
    )
