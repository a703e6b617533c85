// phongscene: POV-Ray 3.7 scene, classic mapping, from examples/seed_buildup.usda
// Render passes (animation frames): 1.
#version 3.7;
// /World/Camera
camera { perspective location <0.0, 3.0, 10.0> direction <0.0, -0.3071817318430195, -1.396280599286452> right <1.333333333333333, 0.0, 0.0> up <0.0, 0.9766444667050899, -0.2148617826751198> }
global_settings { assumed_gamma 1.0 ambient_light rgb <1.0, 1.0, 1.0> }
background { color rgb <0.0, 0.0, 0.0> }
// /World/Lights/Key
light_source { <-5.0, 8.0, 6.0> color rgb <3.1415927, 3.1415927, 3.1415927> }
// /World/Looks/Ambient/Phong
#declare Material_0 = texture { pigment { rgb <0.8, 0.5, 0.1> } finish { ambient 0.25 diffuse 0.0 } }
// /World/Looks/AmbientDiffuse/Phong
#declare Material_1 = texture { pigment { rgb <0.8, 0.5, 0.1> } finish { ambient 0.25 diffuse 0.19098593 } }
// /World/Looks/AmbientDiffuseSpecular/Phong
#declare Material_2 = texture { pigment { rgb <0.8, 0.5, 0.1> } finish { ambient 0.25 diffuse 0.19098593 phong 0.3 phong_size 20.0 } }
// /World/Looks/Ground/Phong
#declare Material_3 = texture { pigment { rgb <0.5, 0.5, 0.5> } finish { ambient 0.25 diffuse 0.19098593 } }
// /World/Geometry/Ambient
sphere { <-2.3, 1.0, 0.0>, 1.0 texture { Material_0 } }
// /World/Geometry/AmbientDiffuse
sphere { <0.0, 1.0, 0.0>, 1.0 texture { Material_1 } }
// /World/Geometry/AmbientDiffuseSpecular
sphere { <2.3, 1.0, 0.0>, 1.0 texture { Material_2 } }
// /World/Geometry/Ground
mesh2 {
  vertex_vectors { 4,
<-1e1,0,-1e1>,
<-1e1,0,1e1>,
<1e1,0,1e1>,
<1e1,0,-1e1>
  }
  face_indices { 2,
<0,1,2>,<0,2,3>
  }
  texture { Material_3 }
}
