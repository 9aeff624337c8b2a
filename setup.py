from glob import glob

from setuptools import find_packages, setup

package_name = 'pool_sim'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['msg_tests', 'benchmarks']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml') + glob('config/*.rviz')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='pool_sim maintainers',
    maintainer_email='pool_sim@example.com',
    description='Spheres falling through air into a pool of water, as a ROS 2 node.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            # Through executables.py, which takes SIGINT and SIGTERM before any heavy import.
            'pool_sim = pool_sim.ros.executables:pool_sim',
            'depth_keeper = pool_sim.ros.executables:depth_keeper',
        ],
        # pytest finds pool_sim.testing's fixture by itself once pool_sim is installed.
        'pytest11': ['pool_sim = pool_sim.testing'],
    },
)
