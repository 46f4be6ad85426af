/* The simulated farm of bench_farm simulate --film (tests/bench/farm_sim.c). */
#ifndef VF_BENCH_FARM_SIM_H
#define VF_BENCH_FARM_SIM_H

/* Runs the simulation and prints its figures; 0 on success. */
int vf_bench_farm_simulate(const char *vcmfarm, const char *film_path, int workers, double seconds,
                           double iteration_seconds, double encode_seconds);

#endif
