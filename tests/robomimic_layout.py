#!/usr/bin/env python3
"""Reads a diffdagger data set the way robomimic's loaders do with their defaults (h5py, next_obs
loaded, filter keys for the train/valid split, env metadata from /data's env_args) and checks what
they would find. Usage: robomimic_layout.py FILE.hdf5 EPISODES"""
import json
import sys

import h5py
import numpy as np


def main(path, episodes):
    with h5py.File(path, "r") as f:
        env_meta = json.loads(f["data"].attrs["env_args"])
        for key in ("env_name", "type", "env_kwargs"):
            assert key in env_meta, f"env_args lacks '{key}': {env_meta}"
        assert isinstance(env_meta["env_kwargs"], dict)

        # robomimic sorts the demos by the number after 'demo_'
        demos = sorted(f["data"].keys(), key=lambda name: int(name[5:]))
        assert demos == [f"demo_{i}" for i in range(episodes)], demos

        train = [d.decode("utf-8") for d in f["mask/train"][:]]
        valid = [d.decode("utf-8") for d in f["mask/valid"][:]]
        assert not set(train) & set(valid), "a demo is in both train and valid"
        assert sorted(train + valid, key=lambda n: int(n[5:])) == demos, "the split does not cover every demo"
        assert valid, "no validation demos"

        total = 0
        obs_keys = list(f["data/demo_0/obs"].keys())
        for name in demos:
            demo = f["data"][name]
            n = int(demo.attrs["num_samples"])
            total += n
            for k in obs_keys:
                obs = demo["obs"][k][()]
                next_obs = demo["next_obs"][k][()]
                assert obs.shape == next_obs.shape and obs.shape[0] == n, (name, k, obs.shape, next_obs.shape)
                assert np.array_equal(next_obs[:-1], obs[1:]), f"{name}: next_obs/{k} is not obs shifted by one step"
            if "actor" in demo:  # written by DAgger sessions: who acted, an index into its labels
                labels = demo["actor"].attrs["labels"]
                labels = (labels.decode("utf-8") if isinstance(labels, bytes) else labels).split(",")
                assert demo["actor"].shape[0] == n and int(demo["actor"][()].max()) < len(labels), (name, labels)
            for field in ("actions", "rewards", "dones", "intervention"):
                assert demo[field].shape[0] == n, (name, field, demo[field].shape)
            assert demo["dones"][-1] == 1
            source = demo.attrs["source"]
            source = source.decode("utf-8") if isinstance(source, bytes) else source
            assert source in ("expert", "intervention", "robot"), source
        assert total == int(f["data"].attrs["total"]), (total, f["data"].attrs["total"])
    print(f"{path}: {episodes} demos ({len(train)} train, {len(valid)} valid), {total} steps, "
          f"obs keys {obs_keys}, env '{env_meta['env_name']}': reads as robomimic reads it")


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]))
