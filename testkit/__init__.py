"""Support for tests and tools: seeded generators, harnesses and writers (no test logic)."""
