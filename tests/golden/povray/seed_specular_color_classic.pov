// phongscene: POV-Ray 3.7 scene, classic mapping, from examples/seed_specular_color.usda
// Render passes (animation frames): 1.
#version 3.7;
// /World/Camera
camera { perspective location <0.0, 3.0, 10.0> direction <0.0, -0.39355194355397827, -1.7888724706999009> right <1.333333333333333, 0.0, 0.0> up <0.0, 0.9766444667050899, -0.2148617826751198> }
global_settings { assumed_gamma 1.0 ambient_light rgb <1.0, 1.0, 1.0> }
background { color rgb <0.0, 0.0, 0.0> }
// /World/Lights/Key
light_source { <-5.0, 8.0, 6.0> color rgb <3.1415927, 3.1415927, 3.1415927> }
// /World/Looks/WhiteHighlight/Phong
#declare Material_0 = texture { pigment { rgb <0.8, 0.1, 0.1> } finish { ambient 0.25 diffuse 0.19098593 phong 0.5 phong_size 20.0 } }
// /World/Looks/DiffuseColoredHighlight/Phong
#declare Material_1 = texture { pigment { rgb <0.8, 0.1, 0.1> } finish { ambient 0.25 diffuse 0.19098593 phong 0.5 phong_size 20.0 } }
// /World/Looks/Ground/Phong
#declare Material_2 = texture { pigment { rgb <0.5, 0.5, 0.5> } finish { ambient 0.25 diffuse 0.19098593 } }
// /World/Geometry/WhiteHighlight
sphere { <-1.3, 1.0, 0.0>, 1.0 texture { Material_0 } }
// /World/Geometry/DiffuseColoredHighlight
sphere { <1.3, 1.0, 0.0>, 1.0 texture { Material_1 } }
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
  texture { Material_2 }
}
