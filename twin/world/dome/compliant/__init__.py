"""The compliant dome: quasi-static frictional contact on an elastic dome solved at every
increment (twin.world.dome.compliant.physics), from the influence model of
twin.world.dome.compliant.compliance and the contact solver of
twin.world.dome.compliant.contact. `COMPLIANT` is its builder (twin.world.dome.registry)."""

from twin.world.dome.compliant.builder import COMPLIANT, CompliantSettings
from twin.world.dome.compliant.physics import COMPLIANT_LEVELS, PLAIN_SOLID, CompliantParams, CompliantPhysics

__all__ = ["COMPLIANT", "COMPLIANT_LEVELS", "PLAIN_SOLID", "CompliantParams", "CompliantPhysics", "CompliantSettings"]
