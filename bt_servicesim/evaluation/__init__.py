"""Many seeded missions per executive, compared on the same seeds; and the seed's baseline."""
