//! `acc-pmc`: PMC interface trait, board register map, Modbus RTU and CAN links.
