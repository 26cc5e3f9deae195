"""Principal component analysis for the latent initialisation (thesis §6.3)."""

from __future__ import annotations

import torch


def principal_components(data: torch.Tensor, num_components: int) -> torch.Tensor:
    """Scores of the first ``num_components`` principal components ``[N, k]`` of
    ``data [N, D]`` (centred here), by SVD; each component's sign is fixed so that its
    largest-magnitude loading is positive (the result is then unique and reproducible)."""
    centred = data - data.mean(0)
    _, _, right = torch.linalg.svd(centred, full_matrices=False)
    components = right[:num_components]  # [k, D]
    largest = components.abs().argmax(dim=1)
    signs = torch.sign(components[torch.arange(num_components), largest])
    return centred @ (components * signs[:, None]).T
