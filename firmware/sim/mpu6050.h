/* mpu6050.h - an MPU-6050-like IMU on the TWI bus (see mpu6050.c). */
#ifndef VIRTUAL_UNO_MPU6050_H
#define VIRTUAL_UNO_MPU6050_H

#include "json.h"

void mpu6050_attach(void); /* at power-on (circuit_attach) */
void mpu6050_reset(void);  /* its registers to their reset values */

/* control commands (control.c's table) */
void cmd_imu(struct jobj *o, struct sbuf *r);
void cmd_imu_reads(struct jobj *o, struct sbuf *r);

#endif
