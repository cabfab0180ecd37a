"""Waiting in rostest check scripts for state that subscriber callbacks fill under a lock."""
import time

import rospy


def wait_for(lock, pred, timeout, poll=0.02):
    """True once pred() holds (checked holding lock); False after timeout seconds or at
    shutdown."""
    end = time.time() + timeout
    while time.time() < end and not rospy.is_shutdown():
        with lock:
            if pred():
                return True
        time.sleep(poll)
    return False
