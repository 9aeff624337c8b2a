"""The baseline: the seed chapter's object-per-sphere design, ported faithfully in style.

Never used by the product. The chapter's source is not in this repository; this follows the
design its text describes: a PointMass object per sphere holding numpy 3-vectors, an
Environment that loops over them applying gravity, buoyancy (the seed's linear submerged
fraction), drag per medium and the floor, and the seed's semi-implicit Euler.
"""
import math

import numpy as np


class PointMass:
    def __init__(self, mass, radius, position, velocity=(0.0, 0.0, 0.0), drag_coefficient=0.47):
        self.mass = mass
        self.radius = radius
        self.position = np.array(position, dtype=float)
        self.velocity = np.array(velocity, dtype=float)
        self.drag_coefficient = drag_coefficient
        self.force = np.zeros(3)

    @property
    def volume(self):
        return 4.0 / 3.0 * math.pi * self.radius**3

    @property
    def area(self):
        return math.pi * self.radius**2

    def apply_force(self, force):
        self.force += force

    def step(self, dt):
        """Semi-implicit Euler, then the accumulated force is cleared."""
        self.velocity += self.force / self.mass * dt
        self.position += self.velocity * dt
        self.force[:] = 0.0


class Environment:
    def __init__(self, gravity=(0.0, 0.0, -9.81), air_density=1.2, water_density=1000.0,
                 surface_z=0.0, floor_z=-4.0, restitution=0.5):
        self.gravity = np.array(gravity, dtype=float)
        self.air_density = air_density
        self.water_density = water_density
        self.surface_z = surface_z
        self.floor_z = floor_z
        self.restitution = restitution
        self.bodies = []

    def add(self, body):
        self.bodies.append(body)

    def submerged_fraction(self, body):
        depth = self.surface_z - (body.position[2] - body.radius)
        return min(max(depth / (2.0 * body.radius), 0.0), 1.0)

    def apply_forces(self, body):
        fraction = self.submerged_fraction(body)
        body.apply_force(body.mass * self.gravity)
        displaced = (self.water_density * fraction + self.air_density * (1.0 - fraction))
        body.apply_force(-displaced * body.volume * self.gravity)
        speed = np.linalg.norm(body.velocity)
        body.apply_force(-0.5 * displaced * body.drag_coefficient * body.area * speed
                         * body.velocity)

    def handle_floor(self, body):
        if body.position[2] - body.radius < self.floor_z:
            body.position[2] = self.floor_z + body.radius
            if body.velocity[2] < 0.0:
                body.velocity[2] = -self.restitution * body.velocity[2]

    def step(self, dt):
        for body in self.bodies:
            self.apply_forces(body)
            body.step(dt)
            self.handle_floor(body)
