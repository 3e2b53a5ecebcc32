"""Why the coating's step error is first order (issue 39, item 3; docs/validation.md, "The
mode cutoff on a coating"): a one-degree-of-freedom oscillator m u'' + K u = -k u (3 kHz
alone), integrated by central differences with the spring's force k u taken at the end of
the step (implicit, as the massless contact solve takes an element's force), against the
trapezoidal average k (u_{n+1} + 2 u_n + u_{n-1}) / 4 and against the history that the
simulation now adds, k (u_{n+1} - u_n + u_{n-1}): the spring still solved at the end of the
step, its two previous values in the predictor (`CoatingStage` in src/dynamics/simulate).
Prints the amplitude over the last period after 5 ms, relative to the exact undamped
amplitude.

    venv/bin/python python/benches/implicit_spring.py
"""

import numpy as np


def amplitude_error(k_over_k0: float, h: float, scheme: str, duration: float = 5e-3) -> float:
    m, k0 = 1.0, (2 * np.pi * 3e3) ** 2
    k = k_over_k0 * k0
    w = np.sqrt((k0 + k) / m)
    n = int(duration / h)
    u_prev, u = np.cos(-w * h), 1.0  # the exact solution at t = -h and 0
    last_period = n - int(2 * np.pi / w / h) - 2
    peak = 0.0
    for i in range(n):
        if scheme == "implicit":
            u_next = (2 * u - u_prev - h * h / m * k0 * u) / (1 + h * h * k / m)
        elif scheme == "history":
            u_next = (2 * u - u_prev - h * h / m * (k0 * u - k * (u - u_prev))) / (
                1 + h * h * k / m
            )
        else:
            u_next = (2 * u - u_prev - h * h / m * (k0 * u + k * (2 * u + u_prev) / 4)) / (
                1 + h * h * k / (4 * m)
            )
        u_prev, u = u, u_next
        if i > last_period:
            peak = max(peak, abs(u))
    return peak - 1.0


def main() -> None:
    print("| k/K | h (s) | spring at n+1 | trapezoidal average | spring at n+1 with its history |")
    print("| --- | --- | --- | --- | --- |")
    for ratio in [1, 10, 100]:
        for h in [5e-7, 1e-6, 2e-6]:
            a, b, c = (amplitude_error(ratio, h, s) for s in ("implicit", "average", "history"))
            print(f"| {ratio} | {h:.0e} | {a:+.2%} | {b:+.3%} | {c:+.3%} |")


if __name__ == "__main__":
    main()
