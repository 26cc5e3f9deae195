"""A/B: the compiled rollout step called once per time step (current) against K time steps
per compiled call (the state-step path only; cart-pole), optionally with cpp_wrapper."""
import sys, time, torch
torch.set_num_threads(1)
import torch._inductor.config as inductor_config
from runners.bench import time_steps, CARTPOLE
from mcpilco.optim.rollout import ParticleRollout, RolloutResult

original_call = ParticleRollout.__call__
K = 1

def several(self, act, particles, bits, noise, t0):
    out = []
    for k in range(noise.shape[0]):
        particles = self._state_step(act, particles, None if bits is None else bits[k], noise[k], t0 + k)
        out.append(particles)
    return out

def unrolled_call(self, num_particles, dropout, generator, act=None, copies=1):
    model = self.stepping_model()
    self.compiler.forget_graphs_of_earlier_fits(self.model.gp)
    like = {"dtype": self.result_dtype, "device": self.initial_mean.device}
    dim = self.initial_mean.shape[0]
    start = torch.randn(num_particles, dim, generator=generator, **like).to(self.dtype)
    noise = torch.randn(self.horizon, self.model.num_outputs, num_particles, generator=generator, **like).to(self.dtype)
    bits = self.policy.dropout_bits(self.horizon, num_particles, generator) if dropout > 0 else None
    act = self.policy.prepare(dropout, self.dtype) if act is None else act
    particles = model.initial_particles(self.initial_states(start))
    states = [model.physical_state(particles)]
    particles = self._state_step(act, particles, None if bits is None else bits[0], noise[0], 0)
    states.append(model.physical_state(particles))
    t = 1
    while t < self.horizon:
        k = min(K, self.horizon - t)
        outs = self.compiler.run(several, True, self, act, particles, None if bits is None else bits[t:t+k], noise[t:t+k], t)
        states.extend(model.physical_state(p) for p in outs)
        particles = outs[-1]
        t += k
    trajectory = torch.stack(states).to(self.result_dtype)
    step_costs = self.cost(trajectory).mean(-1)
    return RolloutResult(step_costs.sum(), step_costs, trajectory)

dtype, n, order = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(",")
cpp = len(sys.argv) > 4 and sys.argv[4] == "cpp"
inductor_config.cpp_wrapper = cpp
for variant in order:
    if variant == "A":
        ParticleRollout.__call__ = original_call
    else:
        K = int(variant)
        ParticleRollout.__call__ = unrolled_call
    torch._dynamo.reset()
    start = time.perf_counter()
    t = time_steps(dtype, n, steps=15, warmup=3, compile=True, setting=CARTPOLE)
    print(f"{time.strftime('%H:%M:%S')} {dtype} n={n} {'current' if variant == 'A' else f'K={K}'} {'cpp_wrapper' if cpp else ''}: median {t.median*1e3:.1f} ms (call incl. compile {time.perf_counter()-start:.0f} s)", flush=True)
